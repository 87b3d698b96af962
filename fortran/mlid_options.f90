!> Estimator and integration options, and their flat encoding.
!>
!> The flat interface carries options as iopt(12) and ropt(12) so that f2py
!> and the deck reader need no derived types; this module is the one place
!> that knows the layout.
module mlid_options
  use mlid_kinds, only: wp, MLID_OK, MLID_ERR_INPUT
  implicit none
  private
  public :: options_t, options_from_flat, options_to_flat, NOPT

  integer, parameter :: NOPT = 12  !< length of iopt and ropt

  type :: options_t
    integer :: max_iter = 30      !< iopt(1): Newton iterations at most
    integer :: halvings = 5       !< iopt(2): step halvings when the cost rises
    logical :: full_r = .false.   !< iopt(3): 0 diagonal R, 1 full R
    logical :: hold = .false.     !< iopt(4): 0 input linear between samples, 1 zero-order hold
    integer :: substeps = 1       !< iopt(5): RK4 steps per sample interval
    integer :: method = 0         !< iopt(6): 0 output error, 1 filter error (Kalman filter)
    logical :: partials = .true.  !< iopt(7): filter error with covariance/gain partials (eqs 4.32-4.34)
    logical :: steady = .false.   !< iopt(8): filter error with the steady-state gain
    integer :: startup = 0        !< iopt(9): 0 from the given values, 1 equation-error start-up
    integer :: rank_min = 0       !< iopt(10): rank-deficient search from this rank (0: full rank only)
    integer :: rank_max = 0       !< iopt(11): ... up to this rank (0: full rank)
    integer :: rank_rule = 0      !< iopt(12): 0 best rank each iteration (report §4.6 blocks 7-10),
                                  !<   1 staged: converge at each rank, one more direction at a time
    real(wp) :: tol_cost = 1.0e-8_wp  !< ropt(1): |dJ| <= tol_cost*max(1,|J|)
    real(wp) :: tol_step = 1.0e-8_wp  !< ropt(2): |dtheta| <= tol_step*|theta|
    real(wp) :: tol_grad = 1.0e-4_wp  !< ropt(3): sqrt(g' M^-1 g) (step in Cramer-Rao sigmas)
    real(wp) :: rcond = 1.0e-10_wp    !< ropt(4): eigenvalues of M below rcond*max are singular
    real(wp) :: prior_decay = 1.0_wp  !< ropt(5): a priori weights times this each iteration (§4.5.2)
  end type options_t

contains

  !> Encode options in the flat layout (unused slots are zero).
  subroutine options_to_flat(opt, iopt, ropt)
    type(options_t), intent(in) :: opt
    integer, intent(out) :: iopt(NOPT)
    real(wp), intent(out) :: ropt(NOPT)
    iopt = 0
    ropt = 0.0_wp
    iopt(1) = opt%max_iter
    iopt(2) = opt%halvings
    iopt(3) = merge(1, 0, opt%full_r)
    iopt(4) = merge(1, 0, opt%hold)
    iopt(5) = opt%substeps
    iopt(6) = opt%method
    iopt(7) = merge(1, 0, opt%partials)
    iopt(8) = merge(1, 0, opt%steady)
    iopt(9) = opt%startup
    iopt(10) = opt%rank_min
    iopt(11) = opt%rank_max
    iopt(12) = opt%rank_rule
    ropt(1) = opt%tol_cost
    ropt(2) = opt%tol_step
    ropt(3) = opt%tol_grad
    ropt(4) = opt%rcond
    ropt(5) = opt%prior_decay
  end subroutine options_to_flat

  !> Decode and check the flat options.  Zero or negative entries where a
  !> positive value is required are errors; the Python layer and the deck
  !> reader fill in the defaults above.
  subroutine options_from_flat(iopt, ropt, opt, status, msg)
    integer, intent(in) :: iopt(NOPT)
    real(wp), intent(in) :: ropt(NOPT)
    type(options_t), intent(out) :: opt
    integer, intent(out) :: status
    character(len=*), intent(out) :: msg

    status = MLID_ERR_INPUT
    opt%max_iter = iopt(1)
    opt%halvings = iopt(2)
    opt%full_r = iopt(3) == 1
    opt%hold = iopt(4) == 1
    opt%substeps = iopt(5)
    opt%method = iopt(6)
    opt%partials = iopt(7) == 1
    opt%steady = iopt(8) == 1
    opt%startup = iopt(9)
    opt%rank_min = iopt(10)
    opt%rank_max = iopt(11)
    opt%rank_rule = iopt(12)
    opt%tol_cost = ropt(1)
    opt%tol_step = ropt(2)
    opt%tol_grad = ropt(3)
    opt%rcond = ropt(4)
    opt%prior_decay = ropt(5)
    if (opt%max_iter < 0) then
      write (msg, '(a,i0)') 'max_iter must be >= 0, got ', opt%max_iter
    else if (opt%halvings < 0) then
      write (msg, '(a,i0)') 'halvings must be >= 0, got ', opt%halvings
    else if (iopt(3) /= 0 .and. iopt(3) /= 1) then
      write (msg, '(a,i0)') 'noise code must be 0 (diagonal) or 1 (full), got ', iopt(3)
    else if (iopt(4) /= 0 .and. iopt(4) /= 1) then
      write (msg, '(a,i0)') 'input hold code must be 0 (linear) or 1 (zero-order), got ', iopt(4)
    else if (opt%method /= 0 .and. opt%method /= 1) then
      write (msg, '(a,i0)') 'method code must be 0 (output error) or 1 (filter error), got ', iopt(6)
    else if (any(iopt(7:9) /= 0 .and. iopt(7:9) /= 1)) then
      msg = 'partials, steady and startup flags must be 0 or 1'
    else if (opt%substeps < 1) then
      write (msg, '(a,i0)') 'substeps must be >= 1, got ', opt%substeps
    else if (.not. (opt%tol_cost >= 0.0_wp .and. opt%tol_step >= 0.0_wp .and. &
                    opt%tol_grad >= 0.0_wp)) then
      msg = 'tolerances tol_cost, tol_step, tol_grad must be >= 0'
    else if (.not. (opt%rcond > 0.0_wp .and. opt%rcond < 1.0_wp)) then
      msg = 'rcond must lie in (0, 1)'
    else if (opt%rank_min < 0 .or. opt%rank_max < 0) then
      msg = 'rank_min and rank_max must be >= 0'
    else if (opt%rank_rule /= 0 .and. opt%rank_rule /= 1) then
      write (msg, '(a,i0)') 'rank rule code must be 0 (each iteration) or 1 (staged), got ', iopt(12)
    else if (opt%rank_max > 0 .and. opt%rank_max < opt%rank_min) then
      write (msg, '(a,i0,a,i0)') 'rank_max = ', opt%rank_max, ' is below rank_min = ', opt%rank_min
    else if (.not. (opt%prior_decay > 0.0_wp .and. opt%prior_decay <= 1.0_wp)) then
      msg = 'prior_decay must lie in (0, 1]'
    else
      status = MLID_OK
      msg = ''
    end if
  end subroutine options_from_flat

end module mlid_options
