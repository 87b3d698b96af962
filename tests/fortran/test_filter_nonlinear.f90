!> The filter's nonlinear path with the steady-state gain (mlid_filter's
!> linearise_once) on a linear problem: a linear model with its linear flag
!> cleared takes that path (linearised once about x0 and the first input,
!> gain partials from forward differences of whole runs), and must give the
!> linear filter's cost, gradient and information.  No model kind with
!> process noise states a linear problem from Python (equations models have
!> none), hence this test here.
program test_filter_nonlinear
  use mlid_kinds, only: wp, MLID_OK
  use mlid_models, only: model_t, linear_model_t, model_layout, layout_t
  use mlid_model_factory, only: model_create, MODEL_LINEAR
  use mlid_params, only: param_map_t, param_map_create, no_ties
  use mlid_options, only: options_t
  use mlid_filter, only: oe_predict
  use mlid_likelihood, only: likelihood
  use mlid_random, only: rng_t, rng_seed, rng_normal
  use test_checks, only: check, finish, failures
  implicit none

  call test_as_linear('held')
  call test_as_linear('continuous')
  call finish()

contains

  !> A body mode and a first-order gust (tests/test_filter_error.py's
  !> gust_model), held noise correlated with the measurement noise or
  !> continuous noise; 300 samples of a doublet with measurement noise.
  subroutine test_as_linear(noise)
    character(len=*), intent(in) :: noise
    integer, parameter :: nx = 3, nu = 1, ny = 2, nw = 1, nt = 300
    class(model_t), allocatable :: lin, nl
    type(options_t) :: opt
    type(param_map_t) :: pm
    type(layout_t) :: l
    type(rng_t) :: rng
    real(wp), allocatable :: theta(:), t(:), u(:, :), y(:, :), yhat(:, :), yl(:, :), &
                             ga(:), gb(:), fa(:, :), fb(:, :), sc(:)
    integer, allocatable :: isfree(:)
    real(wp) :: ca, cb, rhat(ny, ny)
    integer :: status, j, k, nf
    character(len=256) :: msg

    call model_create(MODEL_LINEAR, nx, nu, ny, nw, [integer ::], [real(wp) ::], lin, status, msg)
    l = model_layout(lin)
    allocate (theta(l%nth), isfree(l%nth))
    theta = 0.0_wp
    isfree = 0
    select type (lin)
    type is (linear_model_t)
      theta(lin%of + 1:lin%of + 9) = [-1.0_wp, 0.4_wp, 0.0_wp, -3.0_wp, -0.8_wp, 0.0_wp, &
                                      -3.0_wp, -0.8_wp, -1.5_wp]        ! F, column-major
      theta(lin%og + 1:lin%og + 3) = [2.0_wp, 0.5_wp, 0.0_wp]
      theta(lin%oh + 1:lin%oh + 6) = [1.0_wp, 0.0_wp, 0.0_wp, 1.0_wp, 0.0_wp, 1.0_wp]
      theta(lin%ogam + 1:lin%ogam + 3) = [0.0_wp, 0.0_wp, 1.0_wp]
      isfree(lin%of + [1, 4, 5, 9]) = 1                                 ! f(1,1) f(1,2) f(2,2) f(3,3)
      isfree(lin%og + 1) = 1
      isfree(lin%oh + 4) = 1                                            ! h(2,2)
    end select
    theta(l%ox0 + 1) = 0.1_wp
    theta(l%oq + 1) = 0.05_wp
    theta(l%or + 1:l%or + 2) = [1.0e-3_wp, 2.0e-3_wp]
    if (noise == 'held') theta(l%os + 2) = 0.004_wp                      ! s(1,2)
    isfree(l%ox0 + 1) = 1
    isfree(l%oq + 1) = 1
    isfree(l%or + 1:l%or + 2) = 1
    if (noise == 'held') isfree(l%os + 2) = 1
    call param_map_create(l, isfree, no_ties(l%nth), pm, status, msg)
    call check(status == MLID_OK, 'parameter map: '//trim(msg))
    nf = pm%nf

    allocate (t(nt), u(nu, nt), y(ny, nt), yhat(ny, nt), yl(ny, nt))
    t = [(0.05_wp*(j - 1), j=1, nt)]
    u(1, :) = merge(1.0_wp, 0.0_wp, t >= 0.5_wp .and. t < 1.0_wp) - &
              merge(1.0_wp, 0.0_wp, t >= 1.0_wp .and. t < 1.5_wp)
    call oe_predict(lin, theta, pm, t, u, opt, y, status, msg)
    call rng_seed(rng, 7)
    do j = 1, nt
      do k = 1, ny
        y(k, j) = y(k, j) + 0.05_wp*rng_normal(rng)
      end do
    end do

    opt%method = 1
    opt%steady = .true.
    opt%partials = .true.
    if (noise == 'continuous') opt%process_noise = 1
    allocate (nl, source=lin)
    nl%linear = .false.
    allocate (ga(nf), gb(nf), fa(nf, nf), fb(nf, nf), sc(nf))
    call likelihood(lin, theta, pm, t, u, y, opt, ca, rhat, yl, status, msg, ga, fa)
    call check(status == MLID_OK, noise//' noise, linear filter: '//trim(msg))
    call likelihood(nl, theta, pm, t, u, y, opt, cb, rhat, yhat, status, msg, gb, fb)
    call check(status == MLID_OK, noise//' noise, nonlinear path: '//trim(msg))
    if (failures() > 0) return
    sc = sqrt([(fa(k, k), k=1, nf)])
    write (*, '(a,3(es9.2,a))') '      cost ', abs(cb/ca - 1), ', gradient ', &
      maxval(abs(gb - ga)/sc), ', information ', maxval(abs(fb - fa)/spread_outer(sc)), &
      ' (differences, gradient and information in units of sqrt(M_kk))'
    ! measured: the same cost to the last bit; gradient and information within
    ! 1.2e-6 and 8.9e-7 (held), 5.5e-5 and 1.1e-5 (continuous): the forward
    ! differences' truncation
    call check(abs(cb/ca - 1.0_wp) < 1.0e-12_wp, noise//' noise: the nonlinear path''s '// &
               'steady-gain cost is the linear filter''s')
    call check(maxval(abs(yhat - yl)) < 1.0e-12_wp, noise//' noise: the same predictions')
    call check(maxval(abs(gb - ga)/sc) < 1.0e-4_wp, noise//' noise: the same gradient '// &
               '(forward differences of whole runs against the Riccati partials)')
    call check(maxval(abs(fb - fa)/spread_outer(sc)) < 1.0e-4_wp, noise//' noise: the same '// &
               'information')
  end subroutine test_as_linear

  pure function spread_outer(s) result(o)
    real(wp), intent(in) :: s(:)
    real(wp) :: o(size(s), size(s))
    integer :: k
    do k = 1, size(s)
      o(:, k) = s*s(k)
    end do
  end function spread_outer

end program test_filter_nonlinear
