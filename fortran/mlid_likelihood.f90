!> Output-error likelihood: residuals, measurement-noise covariance from the
!> residuals, cost, gradient and information matrix (report §4.4, eqs 4.17,
!> 4.30, 4.37 with no process noise).
!>
!>     J = 1/2 sum_j [ nu_j' R^-1 nu_j + ln|R| ],  R = (1/N) sum_j nu_j nu_j'
!>
!> (diagonal of the sample covariance, or all of it).  The gradient and the
!> information matrix are taken with R held at that estimate; at R-hat the
!> gradient equals that of the concentrated cost, so one Newton step on theta
!> and one re-estimate of R make a consistent relaxation.
module mlid_likelihood
  use, intrinsic :: ieee_arithmetic, only: ieee_is_finite
  use mlid_kinds, only: wp, MLID_OK, MLID_ERR_SINGULAR
  use mlid_linalg, only: chol_inverse
  use mlid_models, only: model_t
  use mlid_options, only: options_t
  use mlid_filter, only: oe_predict
  implicit none
  private
  public :: oe_likelihood

contains

  !> Cost at theta; with grad and info present also the gradient dJ/dtheta
  !> and the information matrix for the free parameters.
  subroutine oe_likelihood(m, theta, ifree, t, u, y, opt, cost, rhat, yhat, status, msg, &
                           grad, info)
    class(model_t), intent(in) :: m
    real(wp), intent(in) :: theta(:)
    integer, intent(in) :: ifree(:)
    real(wp), intent(in) :: t(:), u(:, :), y(:, :)
    type(options_t), intent(in) :: opt
    real(wp), intent(out) :: cost
    real(wp), intent(out) :: rhat(:, :)
    real(wp), intent(out) :: yhat(:, :)
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg
    real(wp), intent(out), optional :: grad(:)
    real(wp), intent(out), optional :: info(:, :)
    real(wp), allocatable :: dy(:, :, :), nu(:, :), w(:, :)
    real(wp) :: rinv(m%ny, m%ny), logdet, quad
    integer :: ny, nt, nf, j, i, ierr

    ny = m%ny
    nt = size(t)
    nf = size(ifree)
    cost = huge(1.0_wp)
    if (present(grad)) then
      allocate (dy(ny, nf, nt))
      call oe_predict(m, theta, ifree, t, u, opt, yhat, status, msg, dy=dy)
    else
      call oe_predict(m, theta, ifree, t, u, opt, yhat, status, msg)
    end if
    if (status /= MLID_OK) return

    nu = y - yhat
    rhat = matmul(nu, transpose(nu))/nt
    if (.not. opt%full_r) then
      do i = 1, ny
        rhat(:i - 1, i) = 0.0_wp
        rhat(i + 1:, i) = 0.0_wp
      end do
    end if
    do i = 1, ny
      if (.not. (rhat(i, i) > tiny(1.0_wp))) then
        status = MLID_ERR_SINGULAR
        write (msg, '(a,i0,a)') 'residual variance of output ', i, &
          ' is zero or not finite: the output is fitted exactly (noise-free or constant data?)'
        return
      end if
    end do
    call chol_inverse(rhat, rinv, logdet, ierr)
    if (ierr /= 0) then
      status = MLID_ERR_SINGULAR
      msg = 'residual covariance is singular (outputs linearly dependent): use noise = ''diagonal'''
      return
    end if

    quad = sum(nu*matmul(rinv, nu))
    cost = 0.5_wp*(quad + nt*logdet)
    if (.not. ieee_is_finite(cost)) then
      status = MLID_ERR_SINGULAR
      msg = 'cost is not finite'
      return
    end if

    if (present(grad) .and. present(info)) then
      grad = 0.0_wp
      info = 0.0_wp
      allocate (w(ny, nf))
      do j = 1, nt
        w = matmul(rinv, dy(:, :, j))
        grad = grad - matmul(nu(:, j), w)
        info = info + matmul(transpose(dy(:, :, j)), w)
      end do
    end if
  end subroutine oe_likelihood

end module mlid_likelihood
