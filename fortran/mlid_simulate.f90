!> Data generation: the model's outputs along a record plus Gaussian
!> measurement noise from a seeded generator.
module mlid_simulate
  use mlid_kinds, only: wp, MLID_OK, MLID_ERR_INPUT
  use mlid_models, only: model_t
  use mlid_options, only: options_t
  use mlid_filter, only: oe_predict
  use mlid_random, only: rng_t, rng_seed, rng_normal
  implicit none
  private
  public :: simulate_outputs

contains

  !> y(ny, nt) = h(x) + bias + noise_std*N(0,1) along the record;
  !> xhist(nx, nt) receives the states.  Noise is drawn sample by sample,
  !> output by output, from the stream started by seed.
  subroutine simulate_outputs(m, theta, t, u, opt, noise_std, seed, y, xhist, status, msg)
    class(model_t), intent(in) :: m
    real(wp), intent(in) :: theta(:), t(:), u(:, :)
    type(options_t), intent(in) :: opt
    real(wp), intent(in) :: noise_std(:)
    integer, intent(in) :: seed
    real(wp), intent(out) :: y(:, :), xhist(:, :)
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    type(rng_t) :: rng
    integer :: i, j
    integer, allocatable :: nofree(:)

    if (.not. all(noise_std >= 0.0_wp)) then
      status = MLID_ERR_INPUT
      msg = 'noise standard deviations must be finite and >= 0'
      return
    end if
    if (seed < 0) then
      status = MLID_ERR_INPUT
      write (msg, '(a,i0)') 'seed must be >= 0, got ', seed
      return
    end if
    allocate (nofree(0))
    call oe_predict(m, theta, nofree, t, u, opt, y, status, msg, xhist=xhist)
    if (status /= MLID_OK) return
    call rng_seed(rng, seed)
    do j = 1, size(t)
      do i = 1, m%ny
        y(i, j) = y(i, j) + noise_std(i)*rng_normal(rng)
      end do
    end do
  end subroutine simulate_outputs

end module mlid_simulate
